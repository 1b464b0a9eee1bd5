"""usvid.report"""

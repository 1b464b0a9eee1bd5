"""usvid.identify"""

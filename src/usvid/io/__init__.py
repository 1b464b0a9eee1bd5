"""usvid.io"""

"""usvid.prep"""

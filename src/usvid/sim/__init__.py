"""usvid.sim"""

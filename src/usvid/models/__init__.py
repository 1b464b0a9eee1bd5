"""usvid.models"""

"""nlobs.observers"""

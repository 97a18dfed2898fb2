"""nlobs.linear"""

"""nlobs.simulate"""

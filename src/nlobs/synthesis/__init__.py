"""nlobs.synthesis"""

"""nlobs.systems"""

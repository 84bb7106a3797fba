"""prefiltered"""

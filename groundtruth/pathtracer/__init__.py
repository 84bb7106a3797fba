"""pathtracer"""

"""shadow_maps"""

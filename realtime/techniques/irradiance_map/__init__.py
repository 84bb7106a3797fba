"""irradiance_map"""

"""split_sum"""

"""lights"""

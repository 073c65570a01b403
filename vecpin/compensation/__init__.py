"""compensation"""

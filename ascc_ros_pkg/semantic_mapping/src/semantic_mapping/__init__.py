"""Semantic mapping through human activity recognition (thesis chapter 5)."""

"""Foundations shared by every layer: the clock, messages and geometry."""

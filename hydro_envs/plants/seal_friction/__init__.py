"""Measured seal friction of a pneumatic cylinder (measured channels only, no model)."""

"""Gymnasium environments (single and native vector) and the SB3 adapter."""

"""Seeded virtual experiments: synthetic raw logs with a stored, known truth."""

"""Reductions: parsed instrument channels -> the quantities the thesis reports."""

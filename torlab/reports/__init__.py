"""Figures and reports: what users put in papers.

Figures are made with matplotlib on the non-interactive Agg backend, imported
lazily (:func:`torlab.reports.plotting.pyplot`).  Every axis carries a label
with its unit.
"""

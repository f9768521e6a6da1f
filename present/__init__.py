"""Presentation: what people read and look at, made from the studies' results.

Text and numbers (:mod:`formatting`: units read from the quantity names, values rounded to their
standard errors), the diagnosis report as text, JSON and a self-contained HTML file
(:mod:`train_report`, :mod:`page`, its figures as SVG by :mod:`svg`), and the rerun recordings with their
blueprints (:mod:`recording`).
Nothing here simulates or fits.
"""

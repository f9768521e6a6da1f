"""Readers for measured data sets (documented file layouts, checked on entry)."""

from .silverbox import SilverboxData, SilverboxError, load_silverbox

__all__ = ["SilverboxData", "SilverboxError", "load_silverbox"]

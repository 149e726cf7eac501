"""Visualisation: offline HTML recordings (:func:`record_html`) and a non-blocking :class:`LiveViewer`."""

from wbc.viz.live import LiveViewer, RealTimePacer
from wbc.viz.live_overlays import LiveOverlays
from wbc.viz.recording import Polygon, record_html

__all__ = ["LiveOverlays", "LiveViewer", "Polygon", "RealTimePacer", "record_html"]

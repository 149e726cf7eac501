"""Visualisation: offline HTML recordings (:func:`record_html`) and a non-blocking :class:`LiveViewer`.

The names below are imported on first access (PEP 562): ``wbc.viz.progress`` (the progress bar of every run
command) then does not pull in meshcat, Pinocchio's visualizers and their dependencies at start-up.
"""

__all__ = ["LiveOverlays", "LiveViewer", "Polygon", "RealTimePacer", "record_html"]


def __getattr__(name: str):
    if name in ("LiveViewer", "RealTimePacer"):
        from wbc.viz import live as home
    elif name == "LiveOverlays":
        from wbc.viz import live_overlays as home
    elif name in ("Polygon", "record_html"):
        from wbc.viz import recording as home
    else:
        raise AttributeError(f"module 'wbc.viz' has no attribute {name!r}")
    value = getattr(home, name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))

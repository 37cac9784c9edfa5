"""A widget's coarse-then-refine path, as the reader meets it: the pictures after one move of a control."""

import threading


def moved_pictures(monkeypatch, make_panel, control, value):
    """Move ``control(panel)`` of a fresh ``make_panel()`` to ``value``, once with the refinement in the background
    (the worker held until the first picture is taken) and once computed at once.

    Returns ``(first, refined, at_once)``: the PNG bytes of the first picture and of the refined one, and of the
    picture computed at once. Fails if the refinement does not end or leaves an error under the figure."""
    from uwtutor.widgets import _panel

    def moved(background):
        monkeypatch.setattr(_panel, "REFINE_IN_BACKGROUND", background)
        panel = make_panel()
        image = panel.children[2].children[0]
        gate = threading.Event()
        panel._uwtutor_refiner.submit(gate.wait)       # the worker held: the first picture is seen as it is
        control(panel).value = value
        first = bytes(image.value)
        gate.set()
        assert _panel.wait_refined(panel, timeout=120.0)
        assert not panel.children[2].children[1].outputs    # no error under the figure
        return first, bytes(image.value)

    first, refined = moved(True)
    _, at_once = moved(False)
    return first, refined, at_once

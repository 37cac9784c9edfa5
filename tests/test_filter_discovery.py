"""Every public filter of ``uwtutor.filters`` is held to the filter protocol by a contract case (issue 27).

The filters are found, not listed: every class of ``uwtutor.filters.__all__`` with ``predict``, ``update`` and
``run`` (the protocol), and every function of it that returns a ``FilterResult``. Each must be built by a case of
``tests/test_filter_contract.py`` (Kalman family) or ``tests/test_filter_contract_pf.py`` (particle filters), or
be named in ``ELSEWHERE`` with the test file that holds it to its equations. A filter added to the package without
a case fails ``test_every_public_filter_has_a_contract_case``.
"""

from __future__ import annotations

import inspect
import pathlib
from types import ModuleType, SimpleNamespace

import pytest

import test_filter_contract as kalman_contract
import test_filter_contract_pf as particle_contract
import uwtutor.filters
from uwtutor.filters import FilterResult

#: Public filters held elsewhere, with the test file that does it (checked to exist and to name the filter).
ELSEWHERE = {
    "run_filter": ("tests/test_filter_contract.py", "the loop every case's run is compared with, not a filter"),
    "robust_range_kf": ("tests/test_robust.py", "paper E's range filter, against the paper's equations and tests"),
    "cascade_kf": ("tests/test_robust.py", "paper E's cascade filter on the fixes, against the paper's equations"),
}


def public_filters(module: ModuleType = uwtutor.filters) -> tuple[set[str], set[str]]:
    """``(classes, functions)``: the names in ``module.__all__`` that are filters."""
    classes, functions = set(), set()
    for name in module.__all__:
        obj = getattr(module, name)
        if isinstance(obj, type):
            if all(callable(getattr(obj, method, None)) for method in ("predict", "update", "run")) \
                    and name != "Filter":
                classes.add(name)
        elif inspect.isfunction(obj):
            returned = inspect.signature(obj).return_annotation
            returned = getattr(module, returned, None) if isinstance(returned, str) else returned
            if isinstance(returned, type) and issubclass(returned, FilterResult):
                functions.add(name)
    return classes, functions


def covered_classes() -> set[str]:
    """The filter classes the two contract files build (every case, batched)."""
    kalman = {type(case.make(True)).__name__ for case in kalman_contract.CASES}
    particle = {type(particle_contract._make(case.name, True)).__name__ for case in particle_contract.CASES}
    return kalman | particle


def covered_functions(monkeypatch: pytest.MonkeyPatch) -> set[str]:
    """The filter functions the contract's functional forms call (recorded by spies in its namespace)."""
    _, functions = public_filters()
    called: set[str] = set()
    for name in functions:
        original = getattr(kalman_contract, name, None)
        if original is None:
            continue

        def spy(*args, _name=name, _original=original, **kwargs):
            called.add(_name)
            return _original(*args, **kwargs)
        monkeypatch.setattr(kalman_contract, name, spy)
    for case in kalman_contract.CASES:
        if case.functional is not None:
            case.functional(False)
    return called


def test_every_public_filter_has_a_contract_case(monkeypatch):
    classes, functions = public_filters()
    missing = sorted((classes - covered_classes()) | (functions - covered_functions(monkeypatch))
                     - set(ELSEWHERE))
    assert not missing, ("public filters with no case in tests/test_filter_contract.py or "
                         "tests/test_filter_contract_pf.py (add one, or a reason to ELSEWHERE): " + ", ".join(missing))


def test_the_filters_held_elsewhere_are_public_and_named_there():
    classes, functions = public_filters()
    root = pathlib.Path(__file__).parent.parent
    for name, (path, _) in ELSEWHERE.items():
        assert name in classes | functions, f"{name} is not a public filter any more: remove it from ELSEWHERE"
        assert name in (root / path).read_text(), f"{path} does not test {name}"


def test_discovery_finds_a_new_filter():
    class NewFilter:
        def predict(self, u=None): ...
        def update(self, z): ...
        def run(self, z, u=None): ...

    def new_filter(z) -> FilterResult: ...

    fake = SimpleNamespace(__all__=["NewFilter", "new_filter", "FilterResult"], NewFilter=NewFilter,
                           new_filter=new_filter, FilterResult=FilterResult)
    assert public_filters(fake) == ({"NewFilter"}, {"new_filter"})
    classes, functions = public_filters()
    assert {"KalmanFilter", "BootstrapParticleFilter", "CooperativeEKF"} <= classes
    assert {"range_only_ekf", "fading_ekf", "extended_kalman_filter"} <= functions

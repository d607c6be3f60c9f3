"""The measured memory limit: the smaller of the kernel's available memory and the room under
RLIMIT_AS, and the refusal of an allocation beyond it."""

from __future__ import annotations

import resource

import pytest

from posgmc import resources
from posgmc.errors import LimitError


def test_the_address_space_limit_bounds_what_is_available(monkeypatch: pytest.MonkeyPatch) -> None:
    virtual = resources._statm(0)
    if virtual is None:
        pytest.skip("no /proc/self/statm here")
    monkeypatch.setattr(resources.resource, "getrlimit",
                        lambda _: (virtual + (100 << 20), resource.RLIM_INFINITY))
    available = resources.available_bytes()
    assert available is not None and available <= 100 << 20
    with pytest.raises(LimitError) as info:
        resources.check_allocation(200e6, "the thing")
    assert info.value.message.startswith("the thing would need 200.0 MB, but only ")
    resources.check_allocation(1e6, "a small thing")  # fits


def test_nothing_is_refused_where_nothing_can_be_measured(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(resources, "available_bytes", lambda: None)
    resources.check_allocation(1e30, "anything")


def test_sizes_for_people() -> None:
    assert [resources.format_bytes(n) for n in (512, 3.2e6, 1.4e9, 2e18)] == [
        "512 B", "3.2 MB", "1.4 GB", "2000.0 PB"]
    assert resources.usable_cpus() >= 1

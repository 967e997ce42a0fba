"""Where independent pieces of work run: here, one after another, or as Ray tasks on a
local or existing Ray cluster (``pip install '.[ray]'`` in a clone).

`fan_out(fn, items)` calls ``fn(item)`` for every item and yields an `Outcome` as each
finishes (on Ray in completion order, here in item order). A call that raises is tried
again up to ``retries`` times, then reported with its error; the other items go on. Ray
itself re-runs a task whose worker process or node died. ``fn`` must be a module-level
function (Ray ships it by reference) and its items and results picklable.

The Ray workers see the caller's ``MUJOCO_GL``, ``PYOPENGL_PLATFORM`` and ``IMIMIC_*``
settings (the clip cache's folder and bound) when this module starts or joins the
cluster; on a cluster every node needs imimic_gym installed (README, "Scale out"). The
workers' own output (rendering progress bars) stays in Ray's logs, not on the caller's
screen: a failed item's error comes back in its `Outcome`.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

__all__ = ["BACKENDS", "BackendError", "Outcome", "fan_out", "ray_session"]

BACKENDS = ("local", "ray")
Item = TypeVar("Item")


class BackendError(RuntimeError):
    """The backend asked for cannot run here (Ray not installed, no cluster at the address)."""


@dataclass(frozen=True)
class Outcome(Generic[Item]):
    """One item's end: its value, or the error of its last attempt (``"Type: message"``)."""

    item: Item
    value: Any = None
    error: str | None = None
    attempts: int = 1

    @property
    def ok(self) -> bool:
        return self.error is None


def _forwarded_environment() -> dict[str, str]:
    return {k: v for k, v in os.environ.items()
            if k.startswith("IMIMIC_") or k in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}


def _import_ray():
    try:
        import ray
    except ImportError as error:
        raise BackendError("the ray backend needs Ray: pip install '.[ray]' in a clone of "
                           "imimic_gym (make setup installs it)") from error
    return ray


class ray_session:
    """Context manager: a Ray connection for the block. Joins a connection this process
    already has as it is; otherwise calls ``ray.init(address)`` (no dashboard) and shuts
    it down afterwards: ``address`` names a cluster ("auto", "ray://host:10001",
    "host:6379"), or None for Ray's default, the Ray that ``ray start`` runs on this
    machine if there is one, else a new local Ray of ``num_cpus`` (default: all CPUs)."""

    def __init__(self, address: str | None = None, num_cpus: int | None = None) -> None:
        self.address, self.num_cpus, self.started = address, num_cpus, False

    def __enter__(self) -> Any:
        ray = _import_ray()
        if not ray.is_initialized():
            kwargs: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False,
                                      "logging_level": logging.WARNING,  # no start-up notes
                                      "runtime_env": {"env_vars": _forwarded_environment()}}
            if self.address is None:
                kwargs["num_cpus"] = self.num_cpus
            try:
                ray.init(address=self.address, **kwargs)
            except (ConnectionError, RuntimeError, ValueError) as error:
                raise BackendError(f"could not start or reach Ray at "
                                   f"{self.address or 'a new local cluster'}: {error}") from error
            self.started = True
        return ray

    def __exit__(self, *exc: object) -> None:
        if self.started:
            _import_ray().shutdown()


def _describe(error: BaseException) -> str:
    cause = getattr(error, "cause", None)  # a RayTaskError carries the task's exception
    if isinstance(cause, BaseException):
        error = cause
    return f"{type(error).__name__}: {error}".strip().splitlines()[0][:500]


def fan_out(fn: Callable[[Item], Any], items: Iterable[Item], backend: str = "local",
            address: str | None = None, retries: int = 1) -> Iterator[Outcome[Item]]:
    """``fn(item)`` for each item on ``backend`` ("local" or "ray"), yielding each
    `Outcome` as it finishes. An item whose call raises is tried ``retries`` more times."""
    if backend not in BACKENDS:
        raise ValueError(f"unknown backend {backend!r}; expected one of {BACKENDS}")
    items = list(items)
    if backend == "local":
        for item in items:
            yield _local(fn, item, retries)
        return
    with ray_session(address) as ray:
        task = ray.remote(num_cpus=1)(fn)
        running = {task.remote(item): (item, 1) for item in items}
        while running:
            [ref], _ = ray.wait(list(running), num_returns=1)
            item, attempt = running.pop(ref)
            try:
                value = ray.get(ref)
            except ray.exceptions.RayError as error:
                if attempt <= retries:
                    running[task.remote(item)] = (item, attempt + 1)
                    continue
                yield Outcome(item, error=_describe(error), attempts=attempt)
            else:
                yield Outcome(item, value=value, attempts=attempt)


def _local(fn: Callable[[Item], Any], item: Item, retries: int) -> Outcome[Item]:
    for attempt in range(1, retries + 2):
        try:
            return Outcome(item, value=fn(item), attempts=attempt)
        except Exception as error:
            last = _describe(error)
    return Outcome(item, error=last, attempts=retries + 1)

"""A clock for tests of paced loops: time passes only when the code sleeps or the test
says so, so pacing is checked by value and no test waits on the wall clock."""


class FakeClock:
    """Stands in for the `time` module where a module uses ``time.perf_counter`` and
    ``time.sleep`` (patch it in as that module's ``time``). Starts at 100 s."""

    def __init__(self) -> None:
        self.now = 100.0
        self.sleeps: list[float] = []

    def perf_counter(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.sleeps.append(seconds)
        self.now += seconds

    def spend(self, seconds: float) -> None:
        """Time the code under test takes, as the test decides."""
        self.now += seconds

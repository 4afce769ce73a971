"""tqdm progress lines of the pipeline: the elapsed time of a long stage and the
continuation's speed range (rank 0 only, :mod:`study.pipeline`)."""
from __future__ import annotations

__all__ = ["StageBar", "ProgressBar"]


class StageBar:
    """Context manager: a tqdm line with the elapsed time of a long stage (mesh, FE
    assembly, eigen-solve), refreshed twice a second by a thread."""

    def __init__(self, desc: str, enabled: bool) -> None:
        self.desc, self.enabled = desc, enabled

    def __enter__(self):
        if not self.enabled:
            return self
        import threading

        from tqdm import tqdm
        self.bar = tqdm(total=1, desc=self.desc, leave=False,
                        bar_format="{desc}: running {elapsed}")
        self.stop = threading.Event()

        def tick() -> None:
            while not self.stop.wait(0.5):
                self.bar.refresh()
        self.thread = threading.Thread(target=tick, daemon=True)
        self.thread.start()
        return self

    def __exit__(self, *exc) -> None:
        if self.enabled:
            self.stop.set()
            self.thread.join()
            self.bar.close()


class ProgressBar:
    """tqdm bar over the speed range (furthest speed reached)."""

    def __init__(self, lo: float, hi: float, enabled: bool) -> None:
        self.lo, self.hi = lo, hi
        self.bar = None
        self.best = 0
        if enabled:
            from tqdm import tqdm
            self.bar = tqdm(total=1000, desc="continuation", unit="‰", leave=False,
                            bar_format="{desc}: {percentage:3.0f}%|{bar}| {postfix}")

    def update(self, branch) -> None:
        if self.bar is None or len(branch) == 0:
            return
        rpm = float(branch.rpm[-1])
        pos = int(1000 * (rpm - self.lo) / (self.hi - self.lo))
        if pos > self.best:
            self.bar.update(pos - self.best)
            self.best = pos
        self.bar.set_postfix_str(f"{rpm:.0f} rpm, {len(branch)} pts", refresh=False)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()

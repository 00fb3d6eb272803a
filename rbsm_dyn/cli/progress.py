"""Progress of a run on stderr (Progress): a bar on a terminal, log lines in
batch, nothing with --quiet; RBSM_PROGRESS overrides the choice."""
import os
import sys
import time


class Progress:
    """Progress of a run on stderr: a tqdm bar on a terminal, a log line at a
    sane rate in batch (no terminal: every LOG_SECONDS and LOG_FRACTION of
    the run, whichever comes later), nothing with --quiet.  RBSM_PROGRESS
    overrides the choice: ``bar`` (or ``1``) a bar even without a terminal,
    ``log`` lines even on one, ``0`` or ``off`` nothing.

    The ETA counts from the end of the first chunk of steps (which holds
    the compilation of a cold start), not from the start.  A static run by
    relaxation counts whole load steps done; by Newton, whole per cent of
    the load path with the increments done.  ``start(total, dt)`` and
    ``update(n, t, value, label)`` are called by the solvers."""

    LOG_SECONDS = 30.0
    LOG_FRACTION = 0.1

    def __init__(self, enabled, style=None, kind="steps", clock=time.perf_counter):
        """enabled: progress wanted at all (not --quiet); style: "bar", "log"
        or None (from RBSM_PROGRESS and whether stderr is a terminal); kind:
        "steps" (dynamic), "load steps" (static relaxation), "newton"."""
        self.style = progress_style(style) if enabled else None
        self.kind = kind
        self.clock = clock
        self.bar = None
        self.total = 0
        self.first = None          # (wall time, n) at the end of the first chunk
        self.updates = 0
        self.last_log = None       # (wall time, n) of the last log line
        self.t_start = None

    @property
    def enabled(self):
        return self.style is not None

    def retotal(self, total):
        """A new total (an explicit run whose step changed)."""
        self.total = total
        bar = getattr(self, "bar", None)
        if bar is not None:
            bar.total = total
            bar.refresh()

    def start(self, total, dt):
        self.total = total
        self.t_start = self.clock()
        self.first = None
        self.updates = 0
        self.last_log = (self.t_start, 0)
        if self.style == "bar":
            from tqdm import tqdm
            unit = {"steps": "step", "load steps": "load step", "newton": "%"}[self.kind]
            self.bar = tqdm(total=total, unit=unit, dynamic_ncols=True, file=sys.stderr,
                            mininterval=0.5,
                            bar_format="{l_bar}{bar}| {n_fmt}/{total_fmt} [{elapsed}{postfix}]")

    def _whole(self, n):
        """What the bar counts: whole steps, load steps or per cent."""
        import math
        return int(math.floor(n + 1e-9))

    def eta(self, n, now=None):
        """Seconds left, from the rate since the end of the first chunk
        (None until a second chunk has ended)."""
        now = self.clock() if now is None else now
        if self.first is None or n <= self.first[1] or now <= self.first[0]:
            return None
        rate = (n - self.first[1]) / (now - self.first[0])
        return max(0.0, (self.total - n) / rate)

    #: called once, at the first update (the end of the first chunk)
    on_first = None

    def update(self, n, t, value, label="Ek"):
        if self.on_first is not None:
            hook, self.on_first = self.on_first, None
            hook()
        if self.style is None:
            return
        now = self.clock()
        self.updates += 1
        whole = self._whole(n)
        if self.first is None:
            self.first = (now, n)
        eta = self.eta(n, now)
        what = (f"increment {self.updates}" if self.kind == "newton" else
                f"λ={t:.4g}" if self.kind == "load steps" else f"t={t:.4g}")
        text = f"{what} {label}={value:.3g}"
        if self.bar is not None:
            self.bar.n = whole
            self.bar.set_postfix_str(f"ETA {_duration(eta)}, {text}", refresh=False)
            self.bar.refresh()
            return
        t0, n0 = self.last_log
        if (now - t0 >= self.LOG_SECONDS
                and (n - n0) >= self.LOG_FRACTION * max(self.total, 1e-300)):
            self.last_log = (now, n)
            pct = 100.0 * n / max(self.total, 1e-300)
            count = ("" if self.kind == "newton" else
                     f" ({self.kind[:-1] if self.kind.endswith('s') else self.kind} "
                     f"{whole}/{self.total})")
            print(f"rbsm_dyn: progress {pct:.0f} %{count}, {text}, "
                  f"{_duration(now - self.t_start)} elapsed, ETA {_duration(eta)}",
                  file=sys.stderr, flush=True)

    def note(self, text, restart=False):
        """A line said while the run goes on (above the bar, or among the
        log lines; nothing with --quiet).  ``restart``: the run has gone
        back on its path, so the ETA counts afresh from the next update."""
        if restart:
            self.first = None
        if self.style is None:
            return
        line = f"rbsm_dyn: {text}"
        if self.bar is not None:
            self.bar.write(line, file=sys.stderr)
        else:
            print(line, file=sys.stderr, flush=True)

    def close(self):
        self.on_first = None
        if self.bar is not None:
            self.bar.close()
            self.bar = None


def progress_style(style=None):
    """"bar", "log" or None: ``style`` if given, else RBSM_PROGRESS (bar or
    1, log, 0 or off), else a bar on a terminal and log lines without."""
    if style is None:
        env = os.environ.get("RBSM_PROGRESS", "").strip().lower()
        if env in ("0", "off", "no", "none", "false"):
            return None
        if env == "log":
            return "log"
        if env:
            return "bar"
        return "bar" if sys.stderr.isatty() else "log"
    return style


def _duration(seconds):
    """12 s, 3 min 5 s, 2 h 10 min; ? when unknown."""
    if seconds is None:
        return "?"
    s = int(round(seconds))
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60} s"
    return f"{s // 3600} h {s % 3600 // 60} min"

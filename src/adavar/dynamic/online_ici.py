"""The ICI window live: :func:`adavar.dynamic.ici.ici_schedule` decided as the samples arrive.

:class:`IciTracker` is the part of :class:`adavar.OnlineAdaptive` (``method="ici"``) that
repeats, bit for bit, the offline rule of :mod:`adavar.dynamic.ici` (docs/method.md section 11) on
a record that grows.

What each decision depends on, and when it is final
---------------------------------------------------
* **A centre's intervals** (the candidates' estimates and the chains of the three sides)
  need the samples of its windows: up to ``p + lmax - 1`` (the right ``lmax`` window
  starts at ``p``). The DAVAR engine computes them in units of :func:`adavar.dynamic.ici.ici_block`
  consecutive centres aligned on centre 0 (a unit's values depend on the unit, to the
  last bit), so a unit is computed once, when its last centre's windows have arrived.
* **A centre's side** is pointwise, except where the left and right windows tie but
  disagree: the side of such a centre depends on the whole run of them (the change at the
  largest contrast of the run, :func:`adavar.dynamic.ici.settle_ties`). A run is a few samples at a
  change, but nothing bounds it (a slow ramp of the noise level can extend it): its rows
  are emitted when it closes (the first centre after it that is not in it), or at the end.
* **A change** (``episodes``, default) is found by segmenting the region of an episode of
  split centres (:mod:`adavar.dynamic.ici_episodes`): samples ``first - R .. last + R`` of its
  first and last split centre, ``R = lmax + lmax // 4``
  (:func:`adavar.dynamic.ici_episodes.region_reach`). The episode closes when ``lmax`` centres
  after its last split one are computed with none split (a split centre within ``lmax``
  joins it); its changes and ramps are final once its region is segmented (a region that
  ends in a ramp grows by ``lmax`` at a time: it waits for those samples, and the next
  episode for it). A ramp changes the windows of the centres within ``lmax / 2`` of it,
  which may lie ``R + lmax / 2`` before the episode's first split centre: rows wait until
  no open, queued, growing or future episode can reach them, that far behind the computed
  centres and the first split centre of any such episode. Without ``episodes``, a change
  at centre ``c`` needs the contrast of the ``lmax`` windows up to ``lmax / 2`` centres
  after ``c`` (and the flag of ``c - 1``).
* **The EDF** (``ici_edf="correlation"``) comes from the correlation of the first
  ``edf_samples`` samples (the offline ``ici_edf_samples``): nothing is decided before
  they have arrived. ``ici_edf="engine"`` needs the whole record's noise type and does
  not run live.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from scipy.ndimage import maximum_filter1d

from adavar.core.errors import AdavarInputError
from adavar.core.settings import ICI_EDF_SAMPLES, ICI_GAMMA
from adavar.dynamic import ici_episodes
from adavar.dynamic.ici import (
    LEFT,
    RIGHT,
    IciNoise,
    change_reach,
    ici_block,
    ici_centre_stats,
    ici_contrast,
    ici_noise,
    ici_options,
    ici_side_parts,
    settle_ties,
    side_windows,
    track_ramps,
)

__all__ = ["ICI_EDF_SAMPLES", "IciTracker"]


class IciTracker:
    """The ICI rule over a growing record (module notes), centre by centre, step 1.

    Parameters
    ----------
    lmax, lmin : int
        Longest and shortest window (samples).
    lengths, taus, gamma, sides, edf
        As ``ici_lengths`` .. ``ici_edf`` of :func:`adavar.adaptive_davar`;
        ``edf="engine"`` is refused.
    edf_samples : int
        Samples the correlation EDF is measured on (the offline ``ici_edf_samples``).
    kurtosis, episodes : bool
        As ``ici_kurtosis`` and ``ici_episodes`` of :func:`adavar.adaptive_davar`.

    Attributes
    ----------
    computed : int
        Centres whose intervals are known (a multiple of the unit until the end).
    emitted : int
        Centres whose window is final and was returned.
    latency : int
        Samples between a centre and its row, outside runs of tied, disagreeing sides and
        episodes: ``ici_block(lmax) + lmax - 2``, plus ``lmax + lmax // 4 + lmax // 2``
        with ``episodes`` (about ``3.3 lmax``).

    Raises
    ------
    AdavarInputError
        A bad option, ``edf="engine"`` or ``edf_samples`` None.
    """

    def __init__(
        self,
        *,
        lmax: int,
        lmin: int,
        lengths: Sequence[int] | np.ndarray | None = None,
        taus: Sequence[int] = (1,),
        gamma: float = ICI_GAMMA,
        sides: str = "both",
        edf: str = "correlation",
        edf_samples: int | None = ICI_EDF_SAMPLES,
        kurtosis: bool = True,
        episodes: bool = True,
    ) -> None:
        if edf == "engine":
            raise AdavarInputError(
                "ici_edf='engine' needs the whole record's noise type and cannot run live: "
                "use ici_edf='correlation' (measured on the first ici_edf_samples samples)"
            )
        if edf_samples is None:
            raise AdavarInputError(
                "ici_edf_samples=None (the whole record) cannot run live: give the samples "
                f"to measure the EDF on (default {ICI_EDF_SAMPLES}) and the same to the "
                "offline pass"
            )
        self.options = ici_options(lmax=lmax, lmin=lmin, lengths=lengths, taus=taus,
                                   gamma=gamma, sides=sides, edf=edf, edf_samples=edf_samples,
                                   kurtosis=kurtosis, episodes=episodes)  # fmt: skip
        self.lmax, self.lmin = int(lmax), int(lmin)
        self.block = ici_block(self.lmax)
        self.reach = change_reach(self.lmax)
        self.both = sides == "both"
        self.episodes = self.both and self.options.episodes
        # a ramp reaches lmax // 2 centres beyond its episode's region, which starts lmax
        # before the episode's first split centre
        self._reach = ici_episodes.region_reach(self.lmax)
        self._hold = self._reach + self.lmax // 2 if self.episodes else 0
        self.latency = self.block + self.lmax - 2 + self._hold
        self.noise: IciNoise | None = None
        self.nu: np.ndarray | None = None
        self.nu_half: np.ndarray | None = None
        # episodes: the open run of split centres [first, last], the closed runs waiting for
        # their region, a region growing (first centre, a, b), where the last region ended,
        # the steps found and not yet returned, the ramps whose rows are not all out
        self._run: list[int] | None = None
        self._queue: list[tuple[int, int]] = []
        self._pending: tuple[int, int, int] | None = None
        self._region_end = 0
        self._found: list[int] = []
        self._episodes: list[ici_episodes.Episode] = []  # steps and ramps not yet taken
        self._ramps: list[ici_episodes.RampModel] = []
        self.computed = 0
        self.emitted = 0
        # centres emitted .. computed - 1: their pointwise side parts
        self._adapted = np.zeros((3, 0), dtype=np.int64)
        self._side = np.zeros(0, dtype=np.int8)
        self._tie = np.zeros(0, dtype=bool)
        self._contrast = np.zeros(0)
        # the lmax windows' contrast of centres base .. computed - 1 (changes)
        self._base = 0
        self._split = np.zeros(0, dtype=bool)
        self._peak_contrast = np.zeros(0)
        self._decided = 0  # centres whose change flag is final
        self._previous_raw = False  # the raw peak flag of centre decided - 1

    @property
    def ready(self) -> bool:
        """Whether the EDF is known (:meth:`set_edf`)."""
        return self.nu is not None

    def set_edf(self, head: np.ndarray) -> None:
        """Measure the EDF (and dispersions) on the record's first samples (at most
        ``edf_samples``)."""
        self.noise = ici_noise(np.ascontiguousarray(head, dtype=np.float64), self.options)
        self.nu, self.nu_half = self.noise.nu, self.noise.nu_half

    def oldest_sample(self) -> int:
        """The first sample a later :meth:`advance` reads (before: may be dropped)."""
        return min(self.computed, self.emitted) - self.lmax

    def advance(
        self, extended: Callable[[int, int, bool], np.ndarray], n: int, final: bool
    ) -> tuple[int, np.ndarray, np.ndarray, list[int]]:
        """Compute the units the ``n`` samples complete and return what became final.

        Parameters
        ----------
        extended : callable
            ``extended(r0, r1, final)``: samples ``r0 .. r1 - 1``, mirrored beyond the ends
            (the right end only when ``final``).
        n : int
            Samples received.
        final : bool
            The record has ended: every centre is decided, runs cut at the end settled.

        Returns
        -------
        first : int
            Centre of the first returned row.
        window, shift : ndarray of int64
            Window and shift of centres ``first ..``, in order.
        changes : list of int
            The changes (samples) that became final.
        """
        if self.nu is None:  # pragma: no cover - internal consistency
            raise AssertionError("internal: the ICI EDF is not set")
        if final:
            k1 = n
        else:
            k1 = max(0, n - self.lmax + 1) // self.block * self.block
        if k1 > self.computed:
            self._compute(extended, self.computed, k1, final)
        if self.episodes:
            self._regions(extended, n, final)
        first = self.emitted
        window, shift = self._emit(final)
        if self.episodes:
            changes, self._found = self._found, []
        else:
            changes = self._changes(final) if self.both else []
        return first, window, shift, changes

    def take_episodes(self) -> list[ici_episodes.Episode]:
        """The steps and ramps found since the last call, in order (``episodes`` only)."""
        taken, self._episodes = self._episodes, []
        return taken

    # ------------------------------------------------------------------ internals

    def _compute(self, extended: Callable, k0: int, k1: int, final: bool) -> None:
        """The intervals of centres ``k0 .. k1 - 1`` (whole units from a unit's start)."""
        r0, r1 = k0 - self.lmax + 1, k1 + self.lmax - 1  # every window of these centres
        ext = np.ascontiguousarray(extended(r0, r1, final), dtype=np.float64)
        centres = np.arange(k0, k1, dtype=np.int64)
        assert self.nu_half is not None
        stats = ici_centre_stats(ext, -r0, centres, self.options, self.nu, self.nu_half)
        if self.both:
            side, tie, _, contrast = ici_side_parts(stats.adapted, stats.lo, stats.hi)
            split, peak_contrast = ici_contrast(*stats.last[LEFT], *stats.last[RIGHT])
            if self.episodes:
                self._scan(np.flatnonzero(split) + k0)
            else:
                self._split = np.concatenate((self._split, split))
                self._peak_contrast = np.concatenate((self._peak_contrast, peak_contrast))
        else:
            side = np.zeros(centres.size, dtype=np.int8)
            tie = np.zeros(centres.size, dtype=bool)
            contrast = np.zeros(centres.size)
        self._adapted = np.concatenate((self._adapted, stats.adapted), axis=1)
        self._side = np.concatenate((self._side, side))
        self._tie = np.concatenate((self._tie, tie))
        self._contrast = np.concatenate((self._contrast, contrast))
        self.computed = k1

    def _scan(self, flagged: np.ndarray) -> None:
        """Extend the open run of split centres by ``flagged`` (increasing); a run closes
        (queued for its region) where the next one is more than ``lmax`` after its last."""
        for c in flagged.tolist():
            if self._run is not None and c - self._run[1] > self.lmax:
                self._queue.append((self._run[0], self._run[1]))
                self._run = None
            if self._run is None:
                self._run = [c, c]
            self._run[1] = c

    def _regions(self, extended: Callable, n: int, final: bool) -> None:
        """Close the open run once no split centre can join it (or at the end), and segment
        the queued regions in order, each grown while it ends in a ramp (it waits for the
        samples it grows into; the next waits for it)."""
        if self._run is not None and (final or self.computed - self._run[1] > self.lmax):
            self._queue.append((self._run[0], self._run[1]))
            self._run = None
        assert self.noise is not None
        keywords = dict(dispersion=self.noise.dispersion, clipped=self.noise.clipped,
                        gamma=self.options.gamma)  # fmt: skip
        total = n if final else None  # the record's length, once known
        while True:
            if self._pending is None:
                if not self._queue:
                    return
                first, last = self._queue.pop(0)
                a = max(0, first - self._reach, self._region_end)
                b = last + self._reach if total is None else min(total, last + self._reach)
                if a >= b:
                    continue
                self._pending = (first, a, b)
            first, a, b = self._pending
            if not final and b > n:  # the region grew beyond the samples received
                return
            b = b if total is None else min(total, b)
            found = ici_episodes.find_episodes(
                np.ascontiguousarray(extended(a, b, final), dtype=np.float64), a, **keywords
            )
            grown = ici_episodes.grown_end(found, b, self.lmax, total)
            if grown is not None:
                self._pending = (first, a, grown)
                continue
            self._pending = None
            self._region_end = max(self._region_end, b)
            self._found += [e.start for e in found if not e.ramp]
            self._episodes += found
            for e in found:
                model = ici_episodes.ramp_model(e, self.lmax, self.lmin // 2) if e.ramp else None
                if model is not None:
                    self._ramps.append(model)

    def _emit(self, final: bool) -> tuple[np.ndarray, np.ndarray]:
        """The rows up to the start of a run of ties still open at the computed end (and,
        with ``episodes``, before what an open or future episode's ramp may reach)."""
        tie = self._tie
        cut = tie.size
        if not final and cut and tie[-1]:
            closed = np.flatnonzero(~tie)
            cut = int(closed[-1]) + 1 if closed.size else 0
        if self.episodes and not final:
            # the first centre of an open, queued or growing episode, or of a future one
            start = min([self.computed] + [q[0] for q in self._queue]
                        + ([self._run[0]] if self._run is not None else [])
                        + ([self._pending[0]] if self._pending is not None else []))  # fmt: skip
            cut = min(cut, max(0, start - self._hold - self.emitted))
            if 0 < cut < tie.size and tie[cut] and tie[cut - 1]:  # not within a run of ties
                closed = np.flatnonzero(~tie[:cut])
                cut = int(closed[-1]) + 1 if closed.size else 0
        if cut == 0:
            return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
        side = self._side[:cut].copy()
        settle_ties(side, tie[:cut], self._contrast[:cut])  # whole runs: none is cut
        window, shift = side_windows(self._adapted[:, :cut], side, self.lmin)
        if self._ramps:
            assert self.nu is not None
            centres = np.arange(self.emitted, self.emitted + cut, dtype=np.int64)
            track_ramps(centres, window, shift, side, self._ramps, self.options, self.nu)
            half = self.lmax // 2  # a ramp whose rows are all out is done
            self._ramps = [m for m in self._ramps if m.episode.end + half >= centres[-1] + 1]
        self._adapted = self._adapted[:, cut:]
        self._side, self._tie = self._side[cut:], tie[cut:]
        self._contrast = self._contrast[cut:]
        self.emitted += cut
        return window, shift

    def _changes(self, final: bool) -> list[int]:
        """The change flags that are final: contrast the largest within ``reach``."""
        reach = self.reach
        d0 = self._decided
        d1 = self.computed if final else max(d0, self.computed - reach)
        if d1 <= d0:
            return []
        base = self._base
        s0 = max(0, d0 - reach)  # the filter's windows of d0 .. d1 - 1, clipped at the ends
        s1 = self.computed if final else d1 + reach
        values = self._peak_contrast[s0 - base : s1 - base]
        top = maximum_filter1d(values, size=2 * reach + 1, mode="nearest")
        here = slice(d0 - base, d1 - base)
        raw = self._split[here] & (self._peak_contrast[here] >= top[d0 - s0 : d1 - s0])
        before = np.concatenate(([self._previous_raw], raw[:-1]))
        peaks = np.flatnonzero(raw & ~before) + d0  # a flat top counts once
        self._previous_raw = bool(raw[-1])
        self._decided = d1
        keep = max(0, d1 - reach) - base  # what the next filter windows read
        self._split, self._peak_contrast = self._split[keep:], self._peak_contrast[keep:]
        self._base += keep
        return peaks.tolist()

# SPDX-License-Identifier: Apache-2.0
"""immtrain's runtime: load a model file's tracker and run it over plots.

Type stubs of the compiled module (bindings/python/immtrain_module.cpp). Units: lengths in the
model's length unit (Tracker.length_unit, "m" or "km"), angles in radians, times in seconds; a scan
k is a whole number and one scan is the model's sample period.
"""
import os
from typing import Any, Callable, Dict, List, Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str
"""The project's version, "MAJOR.MINOR.PATCH"."""
model_schema_version: int
"""The newest model-file schema version this module reads."""

_Path = Union[str, os.PathLike]
_Array = npt.NDArray[np.float64]

class FileError(RuntimeError):
    """A model file that cannot be read: the message names the file and the field."""

class InvalidParameter(ValueError):
    """A bad argument (shape, value): the message names the field, e.g. "plots[3, 0]"."""

class Tracker:
    """A model file's filter driven over scan-indexed or timed plots (two-point start, gaps
    predicted). A tracker is fed either scans (process) or times (process_at)."""

    def process(self, k: int, z: npt.ArrayLike) -> Dict[str, Any]:
        """Feeds the plot z = (z1, z2) of scan k — Cartesian (x, y) in the length unit, or polar
        (range, azimuth in rad), as the model's measurement_kind says. Returns "event", "status",
        "envelope_nis" and "outside_envelope"."""
    def process_at(self, t: float, z: npt.ArrayLike) -> Dict[str, Any]:
        """Feeds the plot z taken at time t (s; times must increase), as process(). A plain IMM
        without a learned schedule predicts over any interval; a model of one sample period takes
        times a whole number of periods after the last plot (within 1 %), refusing others with
        status "interval not positive or not a whole number of the model's sample periods"."""
    def run(self, plots: npt.ArrayLike) -> Dict[str, Any]:
        """Runs an (N, 3) array of k, z1, z2 (the GIL released while it runs). Returns per row:
        "k", "event" (list of str), "mean" (N, n), "covariance" (N, n, n), "mode_probabilities"
        (N, m), "envelope_nis" (N,) and "outside_envelope" (N,); NaN before the track starts."""
    def state(self) -> Tuple[_Array, _Array]:
        """The combined mean (n,) and covariance (n, n), in state_names' order and units."""
    def mode_probabilities(self) -> _Array:
        """The mode probabilities (m,), in mode_names' order."""
    @property
    def initialized(self) -> bool:
        """Whether the track has started (after its second plot)."""
    @property
    def kind(self) -> str:
        """The model kind, e.g. "plain_imm"."""
    @property
    def length_unit(self) -> str:
        """The model's length unit, "m" or "km"."""
    @property
    def measurement_covariance(self) -> _Array:
        """R (2, 2): Cartesian in length², polar in (length, rad)²."""
    @property
    def measurement_kind(self) -> str:
        """"cartesian" or "polar"."""
    @property
    def mode_count(self) -> int:
        """The number of modes m."""
    @property
    def mode_names(self) -> List[str]:
        """The modes' names."""
    @property
    def regime(self) -> str:
        """The regime the model was trained for."""
    @property
    def sample_period(self) -> float:
        """T, s: one scan."""
    @property
    def state_dimension(self) -> int:
        """The state dimension n."""
    @property
    def state_names(self) -> List[str]:
        """The state's entries, e.g. ["x", "vx", "y", "vy"] (lengths, length/s, length/s², rad/s)."""

class TrackBank:
    """Many tracks of one model stepped by one call (every kind load_tracker reads)."""

    def __init__(self, path: _Path, capacity: int) -> None:
        """A bank of `capacity` tracks of the model file at `path`; raises FileError."""
    def initialize(self, track: int, mean: npt.ArrayLike, covariance: npt.ArrayLike) -> None:
        """Starts track `track` at mean (n,) with covariance (n, n), finite, the covariance
        symmetric with a non-negative diagonal: what Filter.initialize takes; InvalidParameter
        naming the field otherwise, and nothing changes."""
    def step(self, plots: npt.ArrayLike) -> List[str]:
        """One scan of tracks 0 … N − 1: plots (N, 2), N ≤ capacity, one row per track (NaN: no
        plot). Returns each track's status ("ok" or why its state was left unchanged); the GIL is
        released. InvalidParameter for more rows than tracks."""
    def set_interval(self, dt: float) -> bool:
        """Makes the following steps of every track span dt seconds (a plain IMM without a noise
        schedule: F, Q and mode transitions of the interval). False, and nothing changed, for a
        model of one sample period (step it once per period, with NaN plots between) or a dt
        outside 1 µs to 10 h."""
    def estimate(self, track: int) -> Tuple[_Array, _Array]:
        """Track `track`'s combined mean (n,) and covariance (n, n)."""
    def mode_probabilities(self, track: int) -> _Array:
        """Track `track`'s mode probabilities (m,)."""
    def candidate_log_likelihoods(
        self, plots: npt.ArrayLike, tracks: int, gate: float = ...
    ) -> _Array:
        """The gating matrix (tracks, M): log p(z | track) of each candidate plot (M, 2) under
        tracks 0 … tracks − 1's one-scan predictions, -inf where the squared distance to the
        collapsed prediction exceeds `gate` (a χ² quantile: 9.21 is 99 % for 2-D plots; the
        default inf scores every pair), NaN for an unusable plot. Changes no track; the GIL is
        released. Every plain IMM answers it (one with noise schedules by trial updates), the input
        estimator, the GA-fuzzy IMM and the FCM-IMM (these two by trial updates), the FIMM and
        the wIMM without
        fusion and with the extended update (the nIMM); a fusing or converting wIMM's bank raises
        RuntimeError, as its filter has no split cycle. A plain IMM whose file carries a
        covariance calibration gates each track at `gate` times its calibrated factor, as its
        one-track filter's candidate_distance does."""
    @property
    def capacity(self) -> int:
        """The number of tracks."""
    @property
    def kind(self) -> str:
        """The model kind."""
    @property
    def calibrated(self) -> bool:
        """True where the bank states its covariances and gate through the model file's
        covariance calibration, as the file's Filter does; False: the model's own (a file without
        a calibration)."""
    @property
    def state_dimension(self) -> int:
        """The state dimension n."""

class Filter:
    """One track's filter of a model file, driven by hand (imm::TrackFilter): initialize it, then
    per scan step(z) — or, for gating and assignment, predict(), any candidate questions (which
    change nothing), then update(z) with the plot chosen or miss(). In that order the numbers are
    step()'s and predict_only()'s to the bit. Where the prediction reads the plot (the learned
    kinds, a noise schedule: predicts_before_the_plot False) a candidate's likelihood is a trial
    update that is not kept, and its distance and predicted_plot() are those of the prediction
    without a plot. A wIMM that fuses the azimuth does not split its cycle (has_split_cycle False)
    and raises
    RuntimeError from predict(), update() and miss(). Plots are in the model's measurement space (Cartesian x, y or
    polar range, azimuth; measurement_kind), in the model's length unit."""

    def __init__(self, path: _Path) -> None:
        """The filter of the model file at `path`; raises FileError naming the field."""
    def initialize(self, mean: npt.ArrayLike, covariance: npt.ArrayLike) -> None:
        """Starts the track at mean (n,) with covariance (n, n), finite, the covariance symmetric
        with a non-negative diagonal; InvalidParameter naming the field ("initial_state",
        "initial_covariance") otherwise."""
    def start(self, first_scan: int, first: npt.ArrayLike, second_scan: int,
              second: npt.ArrayLike) -> bool:
        """Starts the track from two plots (the two-point start load_tracker's Tracker makes:
        position from the second, velocity from the difference); False when they give none."""
    def step(self, z: npt.ArrayLike, dt: Optional[float] = None) -> str:
        """One whole cycle with plot z (2,); its status ("ok" or why nothing changed). dt: the
        seconds since the last cycle (any positive interval where takes_any_interval, else a whole
        number of sample periods within 1 %); None: the filter's interval (its sample period, or
        the last dt given)."""
    def predict_only(self, dt: Optional[float] = None) -> str:
        """One whole cycle without a plot (dt as for step)."""
    def predict(self, dt: Optional[float] = None) -> str:
        """The first half: the prediction dt seconds on (as for step), held until update() or
        miss()."""
    def candidate_log_likelihood(self, z: npt.ArrayLike) -> float:
        """log p(z | past plots) of a candidate plot under the held prediction (NaN without one)."""
    def candidate_distance(self, z: npt.ArrayLike) -> float:
        """The candidate's squared distance to the collapsed predicted plot: the gate's χ²(2)."""
    def candidates(self, plots: npt.ArrayLike) -> Tuple[_Array, _Array]:
        """Both questions for plots (M, 2): log-likelihoods (M,) and squared distances (M,)."""
    def predicted_plot(self) -> Optional[Tuple[_Array, _Array]]:
        """The held prediction's plot (2,) and covariance (2, 2), or None."""
    def update(self, z: npt.ArrayLike) -> str:
        """The second half with plot z; on a status other than "ok" the prediction stays held."""
    def miss(self) -> str:
        """The second half without a plot (a missed detection)."""
    def state(self) -> Tuple[_Array, _Array]:
        """The combined mean (n,) and covariance (n, n); RuntimeError before initialize()."""
    def mode_probabilities(self) -> _Array:
        """The mode probabilities (m,); RuntimeError before initialize()."""
    @property
    def has_split_cycle(self) -> bool:
        """Whether predict(), update() and miss() work (every kind but a wIMM that fuses the azimuth)."""
    @property
    def predicts_before_the_plot(self) -> bool:
        """Whether the prediction does not read the plot (the plain IMM without a noise schedule,
        the input estimator); else a candidate's likelihood is a trial update."""
    @property
    def takes_any_interval(self) -> bool:
        """Whether dt may be any positive interval (the plain IMM without a noise schedule), not
        only whole sample periods."""
    @property
    def state_dimension(self) -> int:
        """The state dimension n."""
    @property
    def kind(self) -> str:
        """The model kind."""
    @property
    def sample_period(self) -> float:
        """T, s: the interval of one scan."""
    @property
    def measurement_kind(self) -> str:
        """ "cartesian" or "polar"."""
    @property
    def measurement_covariance(self) -> _Array:
        """R (2, 2) of the plots."""
    @property
    def calibration(self) -> Optional[Dict[str, Any]]:
        """The covariance calibration the model file carries (docs/model-schema.md): memory,
        nis_cap, start_innovation, start_state, edges, level_innovation, level_state (the tables;
        factors are dimensionless), and where this track stands: plots_used, nis_level (its
        weighted mean NIS), innovation_scale and state_scale (the factors of S and P now). None
        for a file without one. S (predicted_plot, candidate_distance) and P (state) are
        reported calibrated; the likelihoods are the model's own."""

def load_tracker(path: _Path, max_gap: int = 50) -> Tracker:
    """A model file of any kind the runtime reads, as a Tracker; a track not updated for more
    than max_gap scans (1 to 1 000 000) is dropped. Raises FileError naming the field,
    InvalidParameter for a max_gap outside its range."""

def inspect(path: _Path) -> Dict[str, Any]:
    """The model's kind, regime, provenance, units and every parameter."""

def loadable_kinds() -> List[str]:
    """The model kinds load_tracker reads."""

def verify(path: _Path) -> Dict[str, Any]:
    """Checks a model file (every field and the filter it builds); raises FileError."""

# --- The trainer's side (the module immtrain_lab, imported on first use of these names) --------

class Regime:
    """A regime: what a filter is trained and judged for (docs/regimes.md). Lengths in its units,
    times in seconds."""
    @property
    def name(self) -> str: ...
    @property
    def units(self) -> str:
        """The length unit: "m" or "km"."""
    @property
    def sample_period(self) -> float:
        """T, s."""
    @property
    def scans(self) -> int:
        """Scans per track."""
    @property
    def digest(self) -> str:
        """SHA-256 of the regime's text (what model files record)."""
    @property
    def splits(self) -> Dict[str, int]:
        """Tracks per split (training, validation, test) and the seed of the first two."""
    @property
    def cases(self) -> List[str]:
        """The scripted cases' names (one empty name for a random regime)."""
    @property
    def toml(self) -> str:
        """The regime's TOML text: written to a file, the tools read the same regime."""
    def draw(self, split: str = "test", seed: Optional[int] = None,
             runs: Optional[int] = None) -> Dict[str, Any]:
        """A split's tracks as imm-data draws them: truth (tracks, scans, 6: x, vx, ax, y, vy, ay),
        plots (tracks, scans, 2), times (scans,) in s, maneuvering (tracks, scans), case
        (tracks,), with the set's regime, split, seed, sample_period, has_truth and digest.
        seed: the test split's seed (default the regime's splits.seed); runs: how many tracks
        (default the split's size). The GIL is released while drawing."""

def load_regime(path: _Path) -> Regime:
    """Reads and validates a regime file; ValueError naming the file and the key when invalid."""

def regime_from_dict(table: Dict[str, Any], name: str = "<dict>") -> Regime:
    """A regime from a dict shaped like a regime file: nested dicts for its tables ([sensor],
    [splits], …), a list of dicts for [[maneuvers]]. Validated as a file is: ValueError naming
    `name` and the key."""

def evaluate(experiment: str, *, model: Optional[_Path] = None, models: _Path = "models",
             regime: Optional[_Path] = None, runs: Optional[int] = None, seed: int = 1,
             classical: Optional[_Path] = None, truth_tracks: bool = False,
             out: Optional[_Path] = None, **options: Any) -> Dict[str, Any]:
    """Runs an imm-eval experiment — plain-imm, ga-imm, input-estimator, wimm, fcm-imm, fimm —
    with the command's options and defaults, and returns its result: experiment, model, regime,
    runs, seed, dataset_digest, filters (each filter's zeta_p, zeta_v, RMSEs in the regime's
    units, position_nees, nis, the shares of scans inside their 95 % bounds, per-scan errors and
    mode probabilities as arrays), the experiment's paired differences as [estimate, lower,
    upper] (the 95 % paired-bootstrap interval; below 0 the first-named filter is better), table
    (the filters' figures a row each: a pandas.DataFrame where pandas is installed, else a dict
    of columns),
    failures (gates), findings and exit_code (imm-eval's). With `out`, also writes the report's
    files there as imm-eval does, the same numbers as its metrics.json. Own options by keyword:
    data (plain-imm), paper_model (ga-imm), config and gate_on (fimm). The GIL is released while
    it runs. InvalidParameter (a ValueError) naming an unknown experiment or an invalid option
    value, TypeError for an option the experiment does not have, FileError (a RuntimeError) naming
    the file and field for a bad model."""

def rank(baselines: List[_Path], candidates: List[_Path], *, evaluations: List[_Path] = ...,
         regime: Optional[_Path] = None, runs: Optional[int] = None, seed: int = 1,
         out: Optional[_Path] = None, ship: Optional[_Path] = None,
         raw_ship: bool = False) -> Dict[str, Any]:
    """The regime's tracker, as imm-eval rank: tracker, tracker_file, bar, reason, ranking (place,
    filter, file, kind, classical, eligible, zeta_p, zeta_v, verdict, versus_bar), findings and
    exit_code. With `out`, writes tracker.json there; with `ship` (and `out`), writes the winner
    there, calibrated unless raw_ship."""

def train(kind: str, *, config: Optional[_Path] = None, regime: Optional[_Path] = None,
          seed: Optional[int] = None, out: Optional[_Path] = None, threads: Optional[int] = None,
          progress: Union[None, bool, Callable[[str, str], None]] = None) -> Dict[str, Any]:
    """Trains one model exactly as `imm-train <kind>` does — ga, mlp, wimm, fcm, tsk, baseline,
    schedule, or the kind's own name (ga_fuzzy_imm, …) — with the command's defaults for what is
    not given: the same parameters for the same seed. progress(level, message) receives every log
    line while it trains (progress=True: a tqdm bar of them, where tqdm is installed); the GIL is
    released otherwise. Ctrl-C stops the training at its next log line with KeyboardInterrupt, and
    a callback that raises stops it with its exception; no model file is written then. Returns model (the file, None when a
    quality gate kept it from being written), exit_code (imm-train's) and metrics (the training
    metrics written beside the model). ValueError for an unknown kind or an invalid config, naming
    the key."""

def import_recordings(files: List[_Path], *, out: _Path, name: str = "recorded",
                      sensor: str = "cartesian", units: str = "m", sample_period: float = 0.0,
                      tolerance: float = 0.05, scans: int = 0) -> Dict[str, Any]:
    """Imports recorded tracks — CSV files, or folders of them (t in s, the plots, optional truth;
    docs/regimes.md) — into the track set file `out`, as imm-data import does: file, digest,
    recordings, windows, scans, sample_period (s), gap_scans, dropped_scans, repeated_lines (exact
    repeats of a track's line before them, dropped) and the tracks as
    numpy arrays (Regime.draw's keys). sensor: cartesian, polar or range_sensor; units: m or km;
    sample_period: 0 takes the first track's median step; tolerance: of a sample period, for each
    time's place on the grid; scans: per window, 0 the shortest track. InvalidParameter (a
    ValueError) naming a bad option, RuntimeError naming the file, line and column of a bad
    recording."""

def multi_target(models: List[_Path], *, regime: Optional[_Path] = None,
                 targets: Optional[int] = None, pd: List[float] = ..., clutter: List[float] = ...,
                 runs: int = 20, seed: int = 1,
                 out: Optional[_Path] = None) -> List[Dict[str, Any]]:
    """imm-eval multi-target: scenes of several targets of the regime (default: the first
    model's) among Poisson clutter, tracked by the reference GNN tracker with each model on the
    same scenes, every detection probability `pd` with every clutter density `clutter` (mean
    false plots per scan over the region; none given: the regime's [scene]). A dict per
    condition (regime, targets, detection_probability, clutter_per_scan, runs, seed, cutoff,
    models): each model's gospa, localization, missed and false parts (the regime's length
    unit), tracks_started_per_scene, breaks_per_scene, swaps_per_scene, gospa_minus_first
    ([estimate, lower, upper], 95 % paired bootstrap over scenes) and per_scene, or `refused`
    with the reason. With `out`, writes metrics.json there as imm-eval does."""

"""Type stubs of the Rust extension `chassis_mc._core` (python/src/lib.rs). Call it through
the functions of `chassis_mc`, which take paths, TOML text, dicts and tables."""

from typing import Any, Callable, Dict, List, Optional, Tuple

__version__: str
MAX_REALISATIONS: int
MAX_SEED: int
MAX_THREADS: int

class Study:
    """A validated study (from `chassis_mc.load`)."""

    @property
    def name(self) -> str: ...
    @property
    def seed(self) -> int: ...
    @property
    def realisations(self) -> int: ...
    @property
    def origin(self) -> str: ...
    @property
    def dir(self) -> str: ...
    def to_toml(self) -> str: ...
    def identity(self) -> str: ...
    def with_overrides(
        self, realisations: Optional[int] = None, seed: Optional[int] = None
    ) -> Study: ...

class ArrowTable:
    """A table held by the Rust side, read through the Arrow PyCapsule interface."""

    @property
    def num_rows(self) -> int: ...
    def __arrow_c_stream__(self, requested_schema: Optional[object] = None) -> object: ...

class RunOutput:
    summary: ArrowTable
    realisations: Optional[ArrowTable]
    files: List[str]
    reused: int
    computed: int

class FitOutput:
    text: str
    table: ArrowTable
    systematic: Optional[ArrowTable]
    files: List[str]

class CheckOutput:
    text: str
    ms_per_realisation: List[float]
    estimated_seconds: float
    output_bytes: float

class DesignOutput:
    sentence: str
    answer: Optional[float]
    answer_sd: Optional[float]
    estimator: str
    realisations: int
    files: List[str]

def load_study(
    *,
    path: Optional[str] = None,
    text: Optional[str] = None,
    dict: Optional[Dict[str, Any]] = None,
    realisations: Optional[int] = None,
    seed: Optional[int] = None,
    base: Optional[str] = None,
) -> Study: ...
def parses_as_toml(text: str) -> bool: ...
def _study_from_values(values: Dict[str, Any], origin: str, dir: str) -> Study: ...
def _study_from_toml(text: str, origin: str, dir: str) -> Study: ...
def cycles(study: Study, threads: Optional[int] = None) -> List[Tuple[str, ArrowTable]]: ...
def run(
    study: Study,
    out: Optional[str] = None,
    threads: Optional[int] = None,
    figures: bool = True,
    progress: Optional[Callable[[int, int], None]] = None,
    notice: Optional[Callable[[str], None]] = None,
    shard: Optional[Tuple[int, int]] = None,
) -> RunOutput: ...
def summarize(inputs: List[str], out: str, figures: bool = True) -> RunOutput: ...
def check(study: Study, threads: Optional[int] = None) -> CheckOutput: ...
def design(
    study: Study,
    vary: str,
    from_: float,
    to: float,
    target: str,
    out: str,
    estimator: Optional[str] = None,
    threads: Optional[int] = None,
) -> DesignOutput: ...
def fit(
    *,
    path: Optional[str] = None,
    text: Optional[str] = None,
    dict: Optional[Dict[str, Any]] = None,
    out: Optional[str] = None,
    log: Optional[str] = None,
    base: Optional[str] = None,
    log_table: Optional[Tuple[str, Any]] = None,
) -> FitOutput: ...
def simulate_log(
    study: Study, path: Optional[str] = None, realisation: int = 0, force: bool = False
) -> ArrowTable: ...
def main(argv: List[str]) -> int: ...

"""Type stubs of the Rust extension `chassis_mc._core` (python/src/lib.rs). Call it through
the functions of `chassis_mc`, which take paths, TOML text, dicts and tables."""

from typing import Any, Callable, List, Optional, Tuple

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

def load_study(
    kind: str,
    value: Any,
    realisations: Optional[int] = None,
    seed: Optional[int] = None,
    base: Optional[str] = None,
) -> Study: ...
def parses_as_toml(text: str) -> bool: ...
def _study_from_toml(text: str, origin: str, dir: str) -> Study: ...
def write_cycles(study: Study, dir: str) -> List[str]: ...
def run(
    study: Study,
    out: str,
    threads: Optional[int] = None,
    figures: bool = True,
    progress: Optional[Callable[[int, int], None]] = None,
    notice: Optional[Callable[[str], None]] = None,
) -> Tuple[List[str], int, int]: ...
def check(study: Study, threads: Optional[int] = None) -> Tuple[str, List[float], float, float]: ...
def design(
    study: Study,
    vary: str,
    from_: float,
    to: float,
    target: str,
    out: str,
    estimator: Optional[str] = None,
    threads: Optional[int] = None,
) -> Tuple[str, Optional[float], Optional[float], str, int, List[str]]: ...
def fit(
    kind: str, value: Any, out: str, log: Optional[str] = None, base: Optional[str] = None
) -> Tuple[str, List[str]]: ...
def simulate_log(study: Study, path: str, realisation: int = 0, force: bool = False) -> int: ...
def main(argv: List[str]) -> int: ...

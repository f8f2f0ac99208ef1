"""Type stubs of the extension module (see ``sism/__init__.py`` for the documented API)."""

from typing import Any, Dict, List, Optional, Tuple

__version__: str

class Scene:
    """A loaded scene at its image size."""

    @property
    def width(self) -> int: ...
    @property
    def height(self) -> int: ...
    @property
    def triangles(self) -> int: ...
    @property
    def path(self) -> str: ...
    @property
    def light_radius(self) -> float: ...

def algorithms() -> List[Dict[str, Any]]: ...
def load_scene(path: str, width: Optional[int] = None, height: Optional[int] = None) -> Scene: ...
def render(
    scene: Scene,
    algo: str,
    params: Optional[Dict[str, Any]] = None,
    machine: Optional[str] = None,
    progress: bool = False,
) -> Dict[str, Any]: ...
def read_visibility(path: str) -> Tuple[bytes, int, int]: ...
def compare(
    reference: Tuple[bytes, int, int],
    test: Tuple[bytes, int, int],
    scene: Optional[Scene] = None,
    shaded_pngs: Optional[Tuple[str, str]] = None,
) -> Dict[str, Any]: ...
def study(
    scene: Scene,
    machine: str,
    algo: str = "sism",
    cores: Optional[List[int]] = None,
    threads: Optional[List[int]] = None,
    l2_kb: Optional[List[int]] = None,
    params: Optional[Dict[str, Any]] = None,
    progress: bool = False,
) -> List[Dict[str, Any]]: ...
def simd_backend() -> str: ...

"""Path controllers: the original's Turn-Wheels (``vilma_heading``), ``pure_pursuit`` and ``stanley``."""

from vilma.control.path.base import PathController, PathOutput
from vilma.control.path.pure_pursuit import PurePursuit, PurePursuitParams
from vilma.control.path.stanley import Stanley, StanleyParams
from vilma.control.path.vilma_heading import VilmaHeading, VilmaHeadingParams

__all__ = ["PathController", "PathOutput", "PurePursuit", "PurePursuitParams", "Stanley", "StanleyParams",
           "VilmaHeading", "VilmaHeadingParams"]

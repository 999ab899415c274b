"""HoloVolume: realistic volume rendering in mixed reality, as VTK modules.

The VTK modules this package extends must be imported before the wrapped HoloVolume
modules, so that their Python classes exist when ours refer to them.
"""

import vtkmodules  # noqa: F401
import vtkmodules.vtkCommonCore  # noqa: F401
import vtkmodules.vtkCommonDataModel  # noqa: F401
import vtkmodules.vtkCommonExecutionModel  # noqa: F401
import vtkmodules.vtkRenderingCore  # noqa: F401
import vtkmodules.vtkRenderingVolume  # noqa: F401

from .holoImagingDenoise import vtkStereoSpatioTemporalDenoiser  # noqa: F401
from .holoRenderingPathTracing import vtkPathTracedVolumeMapper  # noqa: F401
from .holoIOEnvironment import vtkEnvironmentMapReader  # noqa: F401
from .holoRemoting import vtkHoloLensRemotingOutput  # noqa: F401
from .holoLighting import (  # noqa: F401
    vtkDualFisheyeToEquirectangular,
    vtkEnvironmentSyncedLight,
    vtkPanoramaVideoSource,
)

__all__ = [
    "vtkPathTracedVolumeMapper",
    "vtkStereoSpatioTemporalDenoiser",
    "vtkEnvironmentMapReader",
    "vtkPanoramaVideoSource",
    "vtkDualFisheyeToEquirectangular",
    "vtkEnvironmentSyncedLight",
    "vtkHoloLensRemotingOutput",
]

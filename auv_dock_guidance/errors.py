"""Exception types, one per kind of bad input, so callers can say exactly what went wrong."""


class DockGuidanceError(Exception):
    """Base of every error this package raises on purpose."""


class CameraModelError(DockGuidanceError, ValueError):
    """A camera_info file or message that cannot describe a camera."""


class ImageInputError(DockGuidanceError, ValueError):
    """An image that is missing, unreadable or of a kind the detector cannot use."""


class ConfigError(DockGuidanceError, ValueError):
    """A parameter or configuration value outside what the product accepts."""

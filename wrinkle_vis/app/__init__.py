"""The Qt app: three linked views of the skin, muscles and skull (``wrinkle-vis``)."""

from .session import Session

__all__ = ["Session"]

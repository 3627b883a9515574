"""liecontrol: geometric control of spacecraft on SO(3) and SE(3)."""

__version__ = "0.1.0"

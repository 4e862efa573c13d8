"""S3O on Drake: Symbolic State Space Optimization for long-horizon mobile manipulation."""

__version__ = "0.1.0"

"""The version of svrqp: the one constant that
``pyproject.toml`` reads when the package is built."""

__version__ = "0.1.0"

"""jointid: identify the frequency-dependent dynamic stiffness of elastomeric joints."""

__version__ = "0.1.0"

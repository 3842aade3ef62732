"""repro — reproduce the GMD appendix and EnergyMoGen claims on stand-in HumanML3D-format data."""

__version__ = "0.1.0"

"""smeha: studies around the giant magnetostrictive transducer FMU.

Command-line interface (``smeha``), the paper's data; the studies in :mod:`smeha.studies`.
"""
__version__ = "0.1.0"

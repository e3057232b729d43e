"""smeha: studies around the giant magnetostrictive transducer FMU.

Command-line interface (``smeha``), the paper's data, comparisons and plots.
"""
__version__ = "0.1.0"

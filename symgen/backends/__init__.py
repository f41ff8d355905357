"""Programs made from a derived model: CasADi Functions (``casadi``), standalone C99 (``c``), an
FMI 2.0 FMU (``fmu``) and the LaTeX document of the equations (``latex``)."""

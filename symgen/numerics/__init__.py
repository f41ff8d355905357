"""Running a model: coordinate partition, assembly and consistent start (``mechanism``), the IDAS
runner (``simulate``), the compiled paths (``compiled``, ``csolver``), the quasi-static problem
(18)-(20) (``quasistatic``), modes and linearisation (``modes``), under one solver policy
(``symgen.policy``)."""

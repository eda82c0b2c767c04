"""The robot: the Fetch tasks made and stepped (`fetch`), the package's own multi-step
Push (`multistep`), the simplified state of section V-E (`observations`) and the fast
observation path (`fastobs`).

Layer 2: imports the top-level modules and nothing above."""

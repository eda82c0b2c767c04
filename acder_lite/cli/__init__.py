"""The commands of `python -m acder_lite`: train, eval and the parser (`main`), bench,
diagnose, sweep (Ray, one laptop or a cluster: `sweep`, `cluster`); pack, table, robust
and export are the modules of the layers below, registered here.

Layer 7: imports every layer below it; nothing imports it but `__main__`."""

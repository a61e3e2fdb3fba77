"""Watch a run in Rerun (the optional extra ``viz``): live as a mission runs, or from a recording or an MCAP bag.

Nothing here is imported by the rest of the toolkit: `toolkit.cli` imports `toolkit.view.live` only
for ``nxtnav run --view`` and ``nxtnav view``, so ``rerun`` loads only on that path.
"""

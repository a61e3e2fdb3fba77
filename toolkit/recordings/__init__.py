"""Recordings of runs and what reads them: the recorder (`recorder`), its reading and replay through
other localisers (`reading`, `replay`, `replay_report`, `replay_plots`), time lines (`timeline`),
trajectory errors (`trajectory_scores`) and data taken elsewhere as recordings (`imported`)."""

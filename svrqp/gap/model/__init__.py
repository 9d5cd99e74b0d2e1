"""The given model: the baseline fitted on the train rows and refitted with an effect (:mod:`.baseline`), and the per-run recalibration base fitted on the real rows (:mod:`.recalibration`)."""

"""Optional step 5, the within-real-rows evidence (off by default): discrepancy models fitted on the
real rows themselves (:mod:`.attribute`) and their surrogate tests
(:mod:`.surrogate_tests`); it never enters a transfer shrink or the summary."""

"""Step 4, the transfer evidence: leave-one-unit-out refits of the linear family (:mod:`.linear`),
the effects' columns (:mod:`.candidates`), run-level effects (:mod:`.between`), local effects
(:mod:`.windows`), the surrogates (:mod:`.surrogates`), the ranking and its tests
(:mod:`.ranking`) and the refits of a kernel model's own family (:mod:`.kernel`)."""

"""Step 6, the diagnosis in words: the verdict and the summary (:mod:`.verdict`), the
report's renderings and its writer (:mod:`.report`) and its figures (:mod:`.figures`)."""

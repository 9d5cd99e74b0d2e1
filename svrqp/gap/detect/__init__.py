"""Steps 2 and 3, whether and where: the one-sided gate (:mod:`.gate`), where the error concentrates (:mod:`.localise`), and every input against its train range (:mod:`.inputs`)."""

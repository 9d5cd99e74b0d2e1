"""The diagnosis's results, below every step: the records (:mod:`.records`)
and the report's data and JSON document (:mod:`.document`)."""

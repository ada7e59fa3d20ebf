"""The batch backends' shared vector protocol (:mod:`.common`) and the CPU batch (:mod:`.cpu`)."""

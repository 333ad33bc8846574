"""F-CONFORM-COVERAGE: the values a run exercised (:mod:`.values`) and the variant space every option of
which some item makes a simulator read (:mod:`.variants`)."""

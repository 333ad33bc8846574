"""``agspec diff``: two implementations in lockstep on generated episodes (:mod:`.diff`) and the shrinking of
a divergence to a minimal, replayable counterexample (:mod:`.shrink`)."""

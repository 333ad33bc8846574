"""The one lockstep driver and the comparison it calls (F-CONFORM step 1, F-EVENT-DIFF): every episode agspec
plays against an implementation goes through :mod:`.driver`, with its joint actions from :mod:`.actions`."""

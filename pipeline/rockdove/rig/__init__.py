"""The rock dove's rig as values, no USD: the skeleton (:mod:`.skeleton`), skin weights per part (:mod:`.weights`)
and motions as sampled joint transforms (:mod:`.motions`). ``rockdove.usd.skel`` writes them as UsdSkel."""

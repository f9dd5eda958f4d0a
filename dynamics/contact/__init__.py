"""Contact: geometry (:mod:`.geometry`), its flat arrays and candidate pairs (:mod:`.scene`), the narrow phase
(:mod:`.narrow_phase`) and free bodies (:mod:`.free_bodies`); the user's settings (:mod:`.config`: Contact,
Material), the force law (:mod:`.forces`) and its derivatives (:mod:`.force_derivatives`), a Contact made
concrete for a model and a run's contact in the core (:mod:`.resolve`), the public single-state evaluation
(:mod:`.evaluation`: contact_forces) and the contacts kept per sample (:mod:`.outputs`).  The computations are
the C++ core's (``core/contact/``); these modules check, resolve and document them."""

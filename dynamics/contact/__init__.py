"""Contact: geometry (:mod:`.geometry`), its flat arrays and candidate pairs (:mod:`.scene`), the compiled
narrow phase (:mod:`.narrow_phase`) and free bodies (:mod:`.free_bodies`); the user's settings (:mod:`.config`:
Contact, Material), the force law (:mod:`.forces`), a Contact made concrete for a model and its compiled
evaluation (:mod:`.resolve`), the simulation's calls (:mod:`.calls`), the public single-state evaluation
(:mod:`.evaluation`: contact_forces) and the contacts kept per sample (:mod:`.outputs`)."""

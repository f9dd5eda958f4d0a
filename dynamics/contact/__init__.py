"""Contact: geometry (:mod:`.geometry`), its flat arrays and candidate pairs (:mod:`.scene`), the compiled
narrow phase (:mod:`.narrow_phase`) and free bodies (:mod:`.free_bodies`)."""

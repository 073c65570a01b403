"""Identification: the one likelihood (:mod:`.likelihood`), the bounded solver
(:mod:`.solver`), redundancy (:mod:`.redundancy`), the fit and its report
(:mod:`.fit`, :mod:`.report`), and linearised cross-validation (:mod:`.crossval`)."""

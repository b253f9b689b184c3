"""Direct-to-indirect transfer relighting (``direct_to_indirect``) and its saved precomputations (``store``)."""

"""User studies of generated motion, as in the CCNet paper's §4.5 (Tables 2-4).

- :mod:`.render`: two clips side by side in one video (pyvista off screen, mp4 and gif);
- :mod:`.kit`: the questionnaire folder (page, videos, criteria) and the key kept apart;
- :mod:`.pairs`: question pairs from a CCNet dataset and trained models (real vs generated);
- :mod:`.analysis`: the paper's validity rules, counts, t-tests, Table 3 means, Table 4 ANOVA;
- :mod:`.power`: power and sample sizes of t-tests (scipy's noncentral t);
- :mod:`.paper`: the paper's printed numbers, recomputed and checked.

Nothing here invents participants: the kit collects real answers, the analysis reads them.
"""

"""Human-readable output of camsim results.

Text on the terminal: the run summary (:mod:`camsim.reports.summary`) and the units values
are shown in (:mod:`camsim.reports.display`).

Self-contained interactive HTML pages of result files (``camsim report``): the page builder
(:mod:`camsim.reports.page`) reads the file's kind and hands it to the section builder
registered for that kind (:data:`camsim.reports.page.BUILDERS`); :mod:`camsim.reports.sections`
holds the run, comparison, sweep, study, fit and optimisation builders. Plots are Bokeh with
its runtime inlined (:mod:`camsim.reports.figures`); long traces are reduced for display by a
min/max envelope per screen column (:mod:`camsim.reports.envelope`), so peaks are never lost.
:mod:`camsim.reports.browser` prints a page to PDF through a local Chromium.
"""

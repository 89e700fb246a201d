"""The study: sequences x pipelines, run locally or on Ray, tabulated and charted."""

"""Formula curves: engines that search them, templates, residuals and readable forms."""

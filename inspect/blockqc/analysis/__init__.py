"""§AF analysis: accuracy indicators, adjustment factors, correlation and CCA."""

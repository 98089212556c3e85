"""Rendering results.json into pages people read (HTML now; PDF from the same HTML)."""

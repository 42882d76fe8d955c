"""Paper-style tables (pandas → Markdown/CSV) and figures (matplotlib → PNG)."""

"""The sidebar panels and the extension's preferences."""

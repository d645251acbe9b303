"""The reporting stage, what people read: CLI tables, matplotlib figures and the HTML report."""

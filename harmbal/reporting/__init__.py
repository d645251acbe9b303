"""Stage 7, what people read: CLI tables, matplotlib figures and the HTML report."""

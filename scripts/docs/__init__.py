"""The README's pictures: the labelled feature points (`render_fp_docs`) and the demo close-ups
(`render_demo_closeups`)."""

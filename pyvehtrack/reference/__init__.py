"""The float oracle: NumPy/OpenCV/filterpy implementations written from the papers.

Nothing in here calls the C core. Each function is the specification of its C twin
in executable form; tests compare the two within tolerances stated in LSB, px or IoU."""

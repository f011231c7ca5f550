"""`nonholo animate` / nonholo.animate: placeholder, being written."""


def animate(result, path, **options):
    raise NotImplementedError("nonholo.animate is not written yet")

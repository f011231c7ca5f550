"""`nonholo view` / nonholo.view: placeholder, being written."""


def view(result, path, **options):
    raise NotImplementedError("nonholo.view is not written yet")

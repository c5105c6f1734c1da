"""``mrcheck discrepancies``: CAD parts the photo disagrees with."""

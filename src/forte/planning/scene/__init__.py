"""Planning around the world: a start clear of the scene, re-solves with clearance rows where the
verdict found contact, and a diagnosis that names the body in the way."""

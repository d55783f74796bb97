"""``pkmstiff app``: a local browser app to explore a machine (issue 28 item 3).

The app's logic (what the user chose → the request → the result) is plain Python in :mod:`pkmstiff.app.session`
and the 3-D scene in :mod:`pkmstiff.app.scene`, both testable without a browser; :mod:`pkmstiff.app.ui` is the thin
trame user interface over them (trame, trame-vtk and trame-vuetify: the optional extra ``app``).
"""

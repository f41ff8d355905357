"""The LaTeX document of a scene's derived equations, numbered as in the paper
(``document.latex_document``; the slot guide and the quasi-static problem in their sections)."""

"""The accuracy-versus-cost report: HTML + PNG figures and tables of a scene's sweep."""

"""jointid.studies"""

"""realrobot"""

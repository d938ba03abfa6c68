(a comment)
